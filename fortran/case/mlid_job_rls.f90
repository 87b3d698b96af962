!> The online job's recursive least squares (estimator = 'rls'): equation
!> error on the model's outputs.  A model with no states (nx = 0; kind
!> 'equations' writes one) whose outputs are linear in its free parameters,
!>
!>   y_i(k) - bias_i - h_i(u(k), theta with the free set to 0)
!>        = sum over the free theta_j of output i:  dh_i/dtheta_j (u(k)) theta_j,
!>
!> is one regression per output, its regressors the model's exact partials
!> dh_i/dtheta (the record's channels themselves where h is written so:
!> test case 23's coefficients on alpha, beta, the rates and the surfaces),
!> run sample by sample by mlid_rls.  Each free parameter belongs to the
!> one output it enters.  Each regression has its own P0 (the textbook's
!> Cm regression starts from 1e7 I, the others from 1e6 I).  The cost per
!> sample is each output's a-priori residual y - x' theta(k - 1).
module mlid_job_rls
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_case, only: case_t
  use mlid_models, only: model_t, layout_t, model_layout
  use mlid_model_factory, only: model_create
  use mlid_params, only: free_indices
  use mlid_rls, only: rls_settings_t, rls_run
  use mlid_job_report, only: online_summary_t
  use mlid_memory, only: no_memory
  use mlid_text, only: itoa, es_text
  implicit none
  private
  public :: online_rls

  !> The outputs' values at two points must agree with their linear
  !> prediction to this (relative) for the regression to be exact.
  real(wp), parameter :: LINEAR_TOL = 1.0e-9_wp

contains

  !> Recursive least squares of each output of case c's model on its free
  !> parameters over the record t, u, y, into o (in the order of free).
  subroutine online_rls(c, t, u, y, o, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(online_summary_t), intent(inout) :: o
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    class(model_t), allocatable :: m
    type(layout_t) :: l
    real(wp), allocatable :: d(:, :, :), z(:, :)
    integer, allocatable :: ifree(:), owner(:)
    integer :: nf, n, i, ierr

    call model_create(c%mkind, c%nx, c%nu, c%ny, c%nw, c%iconst, c%rconst, m, status, msg)
    if (status /= MLID_OK) return
    l = model_layout(m)
    ifree = free_indices(c%isfree(1:l%np))
    nf = size(ifree)
    n = size(t)
    allocate (d(c%ny, nf, n), z(c%ny, n), o%est(nf, n), o%sig(nf, n), o%s2(c%ny, n), stat=ierr)
    if (ierr /= 0) then
      call no_memory('the regressions of recursive least squares', &
                     real(c%ny, wp)*(nf + 2)*n + 2.0_wp*nf*n, status, msg)
      return
    end if
    call regressions(c, m, l, ifree, t, u, y, d, z, status, msg)
    if (status == MLID_OK) call owners(c, d, ifree, owner, status, msg)
    if (status /= MLID_OK) return
    o%est = 0.0_wp
    o%sig = 0.0_wp
    do i = 1, c%ny
      call regress(c, i, pack([(ierr, ierr=1, nf)], owner == i), c%theta(ifree), d, z, o, &
                   status, msg)
      if (status /= MLID_OK) return
    end do
    o%t = t
    o%names = c%labels(c%isfree(ifree))
    o%measure = 'a-priori residual'
    o%settings = itoa(n)//' updates of '//itoa(count([(any(owner == i), i=1, c%ny)]))// &
                 ' regressions, forgetting '//trim(adjustl(es_text(c%online_lambda, 12, 5)))
  end subroutine online_rls

  !> d(i, :, k) = dh_i/dtheta of the free parameters and z(i, k) = y_i -
  !> bias_i - h_i with them 0, at each sample k; the outputs checked linear
  !> in them (h at a second point is its linear prediction).
  subroutine regressions(c, m, l, ifree, t, u, y, d, z, status, msg)
    type(case_t), intent(in) :: c
    class(model_t), intent(in) :: m
    type(layout_t), intent(in) :: l
    integer, intent(in) :: ifree(:)
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    real(wp), intent(out) :: d(:, :, :), z(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: p0(l%np), p1(l%np), h0(c%ny), h1(c%ny), x(0)
    integer :: k, i
    p0 = c%theta(1:l%np)
    p0(ifree) = 0.0_wp
    p1 = p0
    p1(ifree) = 1.0_wp + abs(c%theta(ifree))
    associate (bias => c%theta(l%obias + 1:l%obias + c%ny))
      do k = 1, size(t)
        call m%h(t(k), x, u(:, k), p0, h0)
        call m%dhdp(t(k), x, u(:, k), p0, ifree, d(:, :, k))
        call m%h(t(k), x, u(:, k), p1, h1)
        z(:, k) = y(:, k) - bias - h0
        do i = 1, c%ny
          if (abs(h1(i) - h0(i) - dot_product(d(i, :, k), p1(ifree))) > LINEAR_TOL* &
              (abs(h1(i)) + abs(h0(i)) + sum(abs(d(i, :, k)*p1(ifree))))) then
            status = MLID_ERR_INPUT
            msg = 'online: ''rls'' regresses outputs linear in the free parameters; output '// &
                  trim(output_name(c, i))//' is not (sample '//itoa(k)//')'
            return
          end if
        end do
      end do
    end associate
    status = MLID_OK
    msg = ''
  end subroutine regressions

  !> owner(j): the one output free parameter j enters (its partial not
  !> zero throughout the record).
  subroutine owners(c, d, ifree, owner, status, msg)
    type(case_t), intent(in) :: c
    real(wp), intent(in) :: d(:, :, :)
    integer, intent(in) :: ifree(:)
    integer, allocatable, intent(out) :: owner(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    logical :: enters(size(d, 1))
    integer :: j
    allocate (owner(size(ifree)))
    status = MLID_ERR_INPUT
    do j = 1, size(ifree)
      enters = any(d(:, j, :) /= 0.0_wp, dim=2)
      if (count(enters) > 1) then
        msg = 'online: ''rls'' regresses each output on its own parameters; '// &
              trim(c%labels(c%isfree(ifree(j))))//' enters '//itoa(count(enters))//' outputs'
        return
      else if (count(enters) == 0) then
        msg = 'online: ''rls'': '//trim(c%labels(c%isfree(ifree(j))))//' enters no output '// &
              '(its regressor is zero throughout the record)'
        return
      end if
      owner(j) = findloc(enters, .true., 1)
    end do
    status = MLID_OK
    msg = ''
  end subroutine owners

  !> Output i's regression on the free parameters idx (places in the order
  !> of free) from theta0 (of all free), into o's rows idx; its a-priori
  !> residuals into o%s2(i, :).
  subroutine regress(c, i, idx, theta0, d, z, o, status, msg)
    type(case_t), intent(in) :: c
    integer, intent(in) :: i, idx(:)
    real(wp), intent(in) :: theta0(:), d(:, :, :), z(:, :)
    type(online_summary_t), intent(inout) :: o
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(rls_settings_t) :: s
    real(wp), allocatable :: x(:, :), th(:, :), sg(:, :)
    integer :: k, n
    n = size(z, 2)
    if (size(idx) == 0) then             ! nothing free: the model's own prediction error
      o%s2(i, :) = z(i, :)
      status = MLID_OK
      msg = ''
      return
    end if
    s%lambda = c%online_lambda
    s%p_max = c%online_pmax
    if (size(c%online_p0) > 0) s%p0 = c%online_p0(min(i, size(c%online_p0)))
    x = d(i, idx, :)
    allocate (th(size(idx), n), sg(size(idx), n))
    call rls_run(x, z(i, :), theta0(idx), s, th, sg, status, msg)
    if (status /= MLID_OK) then
      msg = 'online: output '//trim(output_name(c, i))//': '//trim(msg)
      return
    end if
    o%est(idx, :) = th
    o%sig(idx, :) = sg
    o%s2(i, 1) = z(i, 1) - dot_product(x(:, 1), theta0(idx))
    do k = 2, n
      o%s2(i, k) = z(i, k) - dot_product(x(:, k), th(:, k - 1))
    end do
  end subroutine regress

  !> Output i's name: &model's, else y<i>.
  function output_name(c, i) result(name)
    type(case_t), intent(in) :: c
    integer, intent(in) :: i
    character(len=:), allocatable :: name
    name = 'y'//itoa(i)
    if (allocated(c%output_names)) then
      if (size(c%output_names) == c%ny) name = trim(c%output_names(i))
    end if
  end function output_name

end module mlid_job_rls
