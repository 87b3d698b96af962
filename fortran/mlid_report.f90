!> The printed report of a fit (report Table 5.3 layout) and the JSON form
!> of a case result.  mlid/result.py prints the same table.
module mlid_report
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, stop_reason_text
  use mlid_linalg, only: chol_inverse
  implicit none
  private
  public :: report_fit, json_open, json_close, json_case

contains

  !> Table of start, estimate and Cramer-Rao sigma per free parameter.
  subroutine report_fit(unit, method, labels, start, est, sig, cost, rhat, niter, reason, converged, &
                        rank, rank_min, eigval, eigvec, cov)
    integer, intent(in) :: unit
    character(len=*), intent(in) :: method
    character(len=*), intent(in) :: labels(:)
    real(wp), intent(in) :: start(:), est(:), sig(:), cost, rhat(:, :)
    integer, intent(in) :: niter, reason, rank, rank_min
    logical, intent(in) :: converged
    real(wp), intent(in) :: eigval(:), eigvec(:, :), cov(:, :)
    integer :: k

    write (unit, '(a,i0,a)') ' '//trim(method)//': ', niter, ' iterations, '// &
      trim(merge('converged    ', 'NOT converged', converged))//' ('// &
      trim(stop_reason_text(reason))//')'
    if (rank_min > 0) write (unit, '(a,i0,a,i0,a)') ' rank-deficient solution: rank ', rank, &
      ' of ', size(labels), ' (sigma from the same rank)'
    write (unit, '(1x,a16,a15,a15,a13)') 'parameter       ', 'start', 'estimate', 'sigma'
    do k = 1, size(labels)
      write (unit, '(1x,a16,2es15.6e2,es13.4e2)') labels(k), start(k), est(k), sig(k)
    end do
    ! output error estimates R; filter error reports the mean innovation covariance B
    write (unit, '(a,es17.10e2,a,es13.6e2)') ' cost J = ', cost, '   det '// &
      trim(merge('R', 'B', method(1:6) == 'output'))//' = ', det_r(rhat)
    write (unit, '(a,*(1x,es10.4e2))') ' '//trim(merge('R diagonal:      ', 'B diagonal (mean)', &
      method(1:6) == 'output')), (rhat(k, k), k=1, size(rhat, 1))
    call report_identifiability(unit, labels, eigval, eigvec, cov)
  end subroutine report_fit

  !> What the information says about the parameters (report §4.5, §5.3.5):
  !> the eigenvalue spread of the normalised information, its weakest
  !> direction as a combination of named parameters, correlations above 0.9.
  subroutine report_identifiability(unit, labels, eigval, eigvec, cov)
    integer, intent(in) :: unit
    character(len=*), intent(in) :: labels(:)
    real(wp), intent(in) :: eigval(:), eigvec(:, :), cov(:, :)
    character(len=:), allocatable :: line
    character(len=16) :: num
    integer :: n, k, l, order(size(eigval)), shown
    real(wp) :: c

    n = size(eigval)
    if (n == 0) return
    line = ' normalised information: eigenvalues '//trim(fmt_e(eigval(1)))//' to '// &
           trim(fmt_e(eigval(n)))
    if (eigval(1) > 0.0_wp) line = line//', spread '//trim(fmt_e(eigval(n)/eigval(1)))
    write (unit, '(a)') line
    ! components of the weakest direction, largest first
    order = [(k, k=1, n)]
    do k = 1, n
      do l = k + 1, n
        if (abs(eigvec(order(l), 1)) > abs(eigvec(order(k), 1))) order([k, l]) = order([l, k])
      end do
    end do
    line = ' weakest direction:'
    shown = 0
    do k = 1, n
      if (abs(eigvec(order(k), 1)) < 0.1_wp .or. shown == 5) exit
      write (num, '(sp,f5.2)') eigvec(order(k), 1)
      line = line//' '//trim(num)//' '//trim(labels(order(k)))
      shown = shown + 1
    end do
    write (unit, '(a)') line
    line = ' correlations above 0.9:'
    shown = 0
    do k = 1, n
      do l = k + 1, n
        if (.not. (cov(k, k) > 0.0_wp .and. cov(l, l) > 0.0_wp)) cycle
        c = cov(k, l)/sqrt(cov(k, k)*cov(l, l))
        if (abs(c) <= 0.9_wp) cycle
        write (num, '(sp,f5.2)') c
        line = line//trim(merge(' ', ',', shown == 0))//' '//trim(labels(k))//'/'//trim(labels(l))// &
               ' '//trim(num)
        shown = shown + 1
      end do
    end do
    if (shown == 0) line = line//' none'
    write (unit, '(a)') line
  end subroutine report_identifiability

  function fmt_e(x) result(s)
    real(wp), intent(in) :: x
    character(len=16) :: s
    write (s, '(es10.3e2)') x
    s = adjustl(s)
  end function fmt_e

  !> det R of the (positive-definite) noise or innovation covariance, from
  !> the Cholesky log-determinant; 0 if it is not positive definite.
  real(wp) function det_r(a)
    real(wp), intent(in) :: a(:, :)
    real(wp) :: ainv(size(a, 1), size(a, 1)), logdet
    integer :: info
    call chol_inverse(a, ainv, logdet, info)
    det_r = 0.0_wp
    if (info == 0) det_r = exp(logdet)
  end function det_r

  subroutine json_open(unit)
    integer, intent(in) :: unit
    write (unit, '(a)') '['
  end subroutine json_open

  subroutine json_close(unit)
    integer, intent(in) :: unit
    write (unit, '(a)') ']'
  end subroutine json_close

  !> One case as a JSON object (the keys mlid run --json writes).
  subroutine json_case(unit, first, title, job, status, msg, labels, est, sig, cost, rhat, &
                       niter, converged, wall)
    integer, intent(in) :: unit
    logical, intent(in) :: first
    character(len=*), intent(in) :: title, job, msg
    integer, intent(in) :: status, niter
    character(len=*), intent(in) :: labels(:)
    real(wp), intent(in) :: est(:), sig(:), cost, rhat(:, :), wall
    logical, intent(in) :: converged
    integer :: k

    if (.not. first) write (unit, '(a)') ','
    write (unit, '(a)') '{"title": '//quote(title)//', "job": '//quote(job)//','
    write (unit, '(a,i0,a)') '"status": ', status, ', "message": '//quote(msg)//','
    write (unit, '(a)', advance='no') '"parameters": ['
    do k = 1, size(labels)
      write (unit, '(a)', advance='no') quote(labels(k))//trim(merge(', ', '  ', k < size(labels)))
    end do
    write (unit, '(a)') '],'
    write (unit, '(a)') '"estimate": '//numbers(est)//','
    write (unit, '(a)') '"sigma": '//numbers(sig)//','
    write (unit, '(a)') '"R": ['
    do k = 1, size(rhat, 1)
      write (unit, '(a)') numbers(rhat(k, :))//trim(merge(',', ' ', k < size(rhat, 1)))
    end do
    write (unit, '(a)') '],'
    write (unit, '(a)') '"det_R": '//number(det_r(rhat))//', "cost": '//number(cost)//','
    write (unit, '(a,i0,a)') '"iterations": ', niter, ', "converged": '// &
      trim(merge('true ', 'false', converged))//', "wall_time_s": '//number(wall)//'}'
  end subroutine json_case

  function quote(s) result(q)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: q
    integer :: k
    q = '"'
    do k = 1, len_trim(s)
      if (s(k:k) == '"' .or. s(k:k) == '\') q = q//'\'
      q = q//s(k:k)
    end do
    q = q//'"'
  end function quote

  function number(x) result(s)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=32) :: buf
    if (ieee_is_finite(x)) then
      write (buf, '(es24.16e3)') x
      s = trim(adjustl(buf))
    else
      s = 'null'
    end if
  end function number

  function numbers(x) result(s)
    real(wp), intent(in) :: x(:)
    character(len=:), allocatable :: s
    integer :: k
    s = '['
    do k = 1, size(x)
      s = s//number(x(k))
      if (k < size(x)) s = s//', '
    end do
    s = s//']'
  end function numbers

end module mlid_report
