!> The model, options and parameter map of a flat call, built and checked
!> once for every estimator and job (the flat interface, mlid_jobs): a message names
!> the offending item.
module mlid_setup
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t, model_layout, layout_t
  use mlid_model_factory, only: model_create
  use mlid_options, only: options_t, options_from_flat
  use mlid_params, only: param_map_t, param_map_create, tie_t
  use mlid_sampling, only: record_check_segments
  use mlid_aero_long, only: aero_long_t, check_longitudinal_record
  use mlid_problem, only: problem_t, problem_needs, PART_MODEL, PART_PARAMS, PART_RECORD, &
                          PART_OPTIONS
  implicit none
  private
  public :: setup, problem_setup

contains

  !> Build the model, options and parameter map and check everything the
  !> estimators assume of their arguments (sizes, free set and ties, finite
  !> parameters, time and data, manoeuvres).
  subroutine setup(mkind, nx, nu, ny, nw, theta, isfree, tie, iconst, rconst, t, u, y, iopt, &
                   ropt, nf, m, opt, pm, status, msg, segstart)
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nf
    real(c_double), intent(in) :: theta(:)
    integer(c_int), intent(in) :: isfree(:), iconst(:)
    type(tie_t), intent(in) :: tie
    real(c_double), intent(in) :: rconst(:), t(:), u(:, :), y(:, :)
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    class(model_t), allocatable, intent(out) :: m
    type(options_t), intent(out) :: opt
    type(param_map_t), intent(out) :: pm
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(c_int), intent(in), optional :: segstart(:)   !< first sample of each manoeuvre
    integer :: k, j, nt
    type(layout_t) :: l

    call model_create(mkind, nx, nu, ny, nw, iconst, rconst, m, status, msg)
    if (status /= MLID_OK) return
    call options_from_flat(iopt, ropt, opt, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    nt = size(t)
    if (present(segstart)) then
      if (size(segstart) < 1) then
        msg = 'at least one manoeuvre (segment) is needed'
        return
      end if
      if (segstart(1) /= 1) then
        msg = 'the first manoeuvre must start at sample 1'
        return
      end if
      do k = 2, size(segstart)
        if (segstart(k) < segstart(k - 1) + 2 .or. segstart(k) > nt - 1) then
          write (msg, '(a,i0,a)') 'manoeuvre ', k - 1, ' has fewer than 2 samples, or '// &
            'the manoeuvre starts are not increasing within the record'
          return
        end if
      end do
      l = model_layout(m, segstart)
    else
      l = model_layout(m)
    end if
    if (size(theta) /= l%nth) then
      write (msg, '(a,i0,a,i0)') 'parameter vector has ', size(theta), &
        ' entries, the model needs ', l%nth
      return
    end if
    call param_map_create(l, isfree, tie, pm, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (pm%nf /= nf) then
      write (msg, '(a,i0,a,i0,a)') 'nf = ', nf, ' but ', pm%nf, ' parameters are free'
      return
    end if
    do k = 1, size(theta)
      if (.not. ieee_is_finite(theta(k))) then
        write (msg, '(a,i0,a)') 'parameter ', k, ' is not finite'
        return
      end if
    end do
    if (nt < 2) then
      write (msg, '(a,i0,a)') 'record has ', nt, ' samples, at least 2 are needed'
      return
    end if
    if (nf > 0 .and. (nt < nf .or. nt*ny <= nf)) then
      write (msg, '(a,i0,a,i0,a)') 'record has ', nt, ' samples for ', nf, &
        ' free parameters: too few to estimate them'
      return
    end if
    do j = 1, nt
      if (.not. ieee_is_finite(t(j))) then
        write (msg, '(a,i0)') 'data: time is not finite at sample ', j
        return
      end if
      if (j > 1) then
        if (.not. t(j) > t(j - 1)) then
          write (msg, '(a,i0,a,g0.6)') 'data: time does not increase at sample ', j, &
            ', t = ', t(j)
          return
        end if
      end if
      do k = 1, nu
        if (.not. ieee_is_finite(u(k, j))) then
          write (msg, '(a,i0,a,i0,a,g0.6,a)') 'data: input ', k, ' is NaN or infinite at sample ', &
            j, ' (t = ', t(j), ')'
          return
        end if
      end do
      do k = 1, ny
        if (.not. ieee_is_finite(y(k, j))) then
          write (msg, '(a,i0,a,i0,a,g0.6,a)') 'data: output ', k, &
            ' is NaN or infinite at sample ', j, ' (t = ', t(j), ')'
          return
        end if
      end do
    end do
    ! a jump in time is two manoeuvres joined: named, for every method
    if (present(segstart)) then
      call record_check_segments(t, segstart, status, msg)
      if (status /= MLID_OK) return
    end if
    status = MLID_OK
    msg = ''
    ! model-specific checks of the record (units); may leave a warning in msg
    select type (m)
    type is (aero_long_t)
      if (any(y /= 0.0_wp)) call check_longitudinal_record(u, y, status, msg)
    end select
  end subroutine setup

  !> setup of a call's problem p (mlid_problem), which must have its model,
  !> parameters, record (each manoeuvre's first sample) and options.
  subroutine problem_setup(p, m, opt, pm, status, msg)
    type(problem_t), intent(in) :: p
    class(model_t), allocatable, intent(out) :: m
    type(options_t), intent(out) :: opt
    type(param_map_t), intent(out) :: pm
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    call problem_needs(p, [PART_MODEL, PART_PARAMS, PART_RECORD, PART_OPTIONS], status, msg)
    if (status /= MLID_OK) return
    call setup(p%mkind, p%nx, p%nu, p%ny, p%nw, p%theta, p%isfree, p%tie, p%iconst, p%rconst, &
               p%t, p%u, p%y, p%iopt, p%ropt, count(p%isfree > 0), m, opt, pm, status, msg, &
               p%segstart)
  end subroutine problem_setup

end module mlid_setup
