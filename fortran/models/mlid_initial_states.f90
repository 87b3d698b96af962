!> The initial state from a record (x0_from): each state that an output
!> measures starts at that output's first sample, or at the mean of its
!> first k samples, less the output's bias, manoeuvre by manoeuvre.  Which
!> output is which state the model says (model_t's measured_states); the
!> others keep their x0.  The deck (&estimate x0_from) and Python's fit
!> both come here, on the record in the units the fit sees.
module mlid_initial_states
  use mlid_kinds, only: wp, msg_len, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  use mlid_model_factory, only: model_create, MODEL_KIND_NAMES
  use mlid_text, only: to_lower
  use mlid_layout, only: layout_table_t, layout_of, manoeuvre_map
  implicit none
  private
  public :: x0_from_record, x0_rule_check, X0_RULES

  !> The rules of x0_from: the first sample, or the mean of the first k.
  character(len=8), parameter :: X0_RULES(2) = [character(len=8) :: 'first', 'mean']

contains

  !> theta (laid out for size(segstart) manoeuvres, manoeuvre_map) with
  !> each manoeuvre's x0 of the measured states from its own samples of y
  !> (ny, samples; segstart(j) the first of manoeuvre j): rule 'first', or
  !> 'mean' of the first k, less that manoeuvre's bias of the output.  A
  !> state two outputs measure takes the first of them.
  subroutine x0_from_record(mkind, nx, nu, ny, nw, iconst, rconst, theta, y, segstart, rule, k, &
                            status, msg)
    integer, intent(in) :: mkind, nx, nu, ny, nw, iconst(:), segstart(:), k
    real(wp), intent(in) :: rconst(:), y(:, :)
    real(wp), intent(inout) :: theta(:)
    character(len=*), intent(in) :: rule
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    class(model_t), allocatable :: m
    type(layout_table_t) :: lt
    integer, allocatable :: map(:), seg(:), which(:)
    logical :: known

    call x0_rule_check(rule, k, status, msg)
    if (status /= MLID_OK) return
    call model_create(mkind, nx, nu, ny, nw, iconst, rconst, m, status, msg)
    if (status == MLID_OK) call layout_of(mkind, nx, nu, ny, nw, iconst, rconst, lt, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    call manoeuvre_map(lt, size(segstart), map, seg)
    if (size(map) /= size(theta) .or. size(y, 1) /= ny .or. any(segstart < 1) .or. &
        any(segstart > size(y, 2))) then
      msg = 'x0_from: the parameters or the record do not fit the model and its manoeuvres'
      return
    end if
    allocate (which(ny))
    call m%measured_states(theta(1:lt%np), which, known)
    if (.not. known) then
      msg = 'x0_from: a model of kind '''//trim(MODEL_KIND_NAMES(mkind))//''' cannot say which '// &
            'output is which state: give x0 (or initial_states) instead'
      return
    end if
    if (all(which == 0)) then
      msg = 'x0_from: no output is one of the states (a row of H that is a unit vector, with '// &
            'D''s row zero; an equations output written as the state''s name)'
      return
    end if
    call set_x0(lt, map, seg, which, y, segstart, merge(1, k, to_lower(rule) == 'first'), theta, &
                status, msg)
  end subroutine x0_from_record

  !> rule one of X0_RULES (in any case); k the samples averaged: >= 1 for
  !> 'mean', none (0) or 1 for 'first'.
  subroutine x0_rule_check(rule_given, k, status, msg)
    character(len=*), intent(in) :: rule_given
    integer, intent(in) :: k
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=len(rule_given)) :: rule
    rule = to_lower(rule_given)
    status = MLID_ERR_INPUT
    if (all(X0_RULES /= rule)) then
      msg = 'x0_from must be '''//trim(X0_RULES(1))//''' or '''//trim(X0_RULES(2))//''', got '''// &
            trim(rule_given)//''''
    else if (rule == 'mean' .and. k < 1) then
      write (msg, '(a,i0)') 'x0_from = ''mean'' needs x0_samples >= 1 (the samples averaged), got ', k
    else if (rule == 'first' .and. k /= 0 .and. k /= 1) then
      msg = 'x0_samples is for x0_from = ''mean'' (''first'' takes the first sample)'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine x0_rule_check

  !> Each manoeuvre's x0 of the states that which names, from the mean of
  !> its first k samples of their outputs less its biases.
  subroutine set_x0(lt, map, seg, which, y, segstart, k, theta, status, msg)
    type(layout_table_t), intent(in) :: lt
    integer, intent(in) :: map(:), seg(:), which(:), segstart(:), k
    real(wp), intent(in) :: y(:, :)
    real(wp), intent(inout) :: theta(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, allocatable :: ix(:), ib(:)
    integer :: j, s, i, a, n, ox, ob, e
    real(wp) :: v
    character(len=msg_len) :: buf

    ox = lt%off(findloc(lt%key, 'x0', 1))
    ob = lt%off(findloc(lt%key, 'bias', 1))
    do j = 1, size(segstart)
      a = segstart(j)
      n = size(y, 2) + 1 - a
      if (j < size(segstart)) n = segstart(j + 1) - a
      if (k > n) then
        status = MLID_ERR_INPUT
        write (buf, '(a,i0,a,i0,a,i0)') 'x0_samples = ', k, ' is more than the ', n, &
          ' samples of manoeuvre ', j
        msg = buf
        return
      end if
      ! this manoeuvre's x0 and bias entries (its own, or the shared ones of one manoeuvre)
      ix = pack([(e, e=1, size(map))], seg == j .and. map > ox .and. &
                map <= ox + lt%rows(findloc(lt%key, 'x0', 1)))
      ib = pack([(e, e=1, size(map))], seg == j .and. map > ob .and. map <= ob + size(which))
      do s = 1, size(ix)
        i = findloc(which, s, 1)
        if (i == 0) cycle
        v = sum(y(i, a:a + k - 1))/k
        if (.not. (abs(v) <= huge(1.0_wp))) then
          status = MLID_ERR_INPUT
          write (buf, '(a,i0,a,i0,a)') 'x0_from: output ', i, '''s first samples of manoeuvre ', j, &
            ' are not finite'
          msg = buf
          return
        end if
        theta(ix(s)) = v - theta(ib(i))
      end do
    end do
    status = MLID_OK
    msg = ''
  end subroutine set_x0

end module mlid_initial_states
